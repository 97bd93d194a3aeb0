//! Embeds every template under `templates/` (minijinja-embed): a new page
//! is one more file there, with no list to keep.

fn main() {
    minijinja_embed::embed_templates!("templates");
}
