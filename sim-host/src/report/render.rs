//! The report as a document (headings and [`Block`]s), rendered to Markdown and to a
//! self-contained HTML page whose figures sit beside it (`figures/...`).

use super::experiment::Block;
use std::fmt::Write as _;

/// A heading and what follows it.
pub struct Section {
    /// 1 = `#`, 2 = `##`, …
    pub level: u8,
    pub title: String,
    pub blocks: Vec<Block>,
}

/// Markdown: tables as pipe tables, figures as links (images live in the report directory,
/// not beside the committed copy in docs/).
pub fn markdown(doc: &[Section]) -> String {
    let mut s = String::new();
    for sec in doc {
        let hashes = "#".repeat(usize::from(sec.level.max(1)));
        let _ = writeln!(s, "{hashes} {}\n", sec.title);
        let mut blocks = sec.blocks.iter().peekable();
        while let Some(b) = blocks.next() {
            match b {
                Block::Para(p) => {
                    let _ = writeln!(s, "{p}\n");
                }
                // A run of figures: one line of links.
                Block::Figure { .. } if matches!(blocks.peek(), Some(Block::Figure { .. })) => {
                    let mut links = vec![b];
                    while let Some(f) = blocks.next_if(|x| matches!(x, Block::Figure { .. })) {
                        links.push(f);
                    }
                    let text: Vec<String> = links
                        .iter()
                        .filter_map(|f| match f {
                            Block::Figure { file, caption } => Some(format!("[{caption}](figures/{file})")),
                            _ => None,
                        })
                        .collect();
                    let _ = writeln!(s, "Figures: {}\n", text.join(" · "));
                }
                Block::Table { header, rows } => {
                    let cell = |c: &String| c.replace('|', "\\|").replace('\n', " ");
                    let _ = writeln!(s, "| {} |", header.iter().map(cell).collect::<Vec<_>>().join(" | "));
                    let _ = writeln!(s, "|{}", "---|".repeat(header.len()));
                    for r in rows {
                        let _ = writeln!(s, "| {} |", r.iter().map(cell).collect::<Vec<_>>().join(" | "));
                    }
                    s.push('\n');
                }
                Block::Figure { file, caption } => {
                    let _ = writeln!(s, "Figure: [{caption}](figures/{file})\n");
                }
            }
        }
    }
    s
}

fn escape(t: &str) -> String {
    t.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// Inline Markdown-light: `code`, **bold**, [text](url) — enough for the report's prose.
fn inline(t: &str) -> String {
    let t = escape(t);
    let mut out = String::new();
    let mut code = false;
    let mut bold = false;
    let mut rest = t.as_str();
    while let Some(c) = rest.chars().next() {
        if c == '`' {
            out.push_str(if code { "</code>" } else { "<code>" });
            code = !code;
            rest = &rest[1..];
        } else if !code && rest.starts_with("**") {
            out.push_str(if bold { "</strong>" } else { "<strong>" });
            bold = !bold;
            rest = &rest[2..];
        } else if !code && c == '[' {
            // [text](url)
            let link = rest.find("](").and_then(|m| rest[m..].find(')').map(|e| (m, m + e)));
            match link {
                Some((m, e)) if !rest[1..m].contains('[') => {
                    let _ = write!(out, "<a href=\"{}\">{}</a>", &rest[m + 2..e], &rest[1..m]);
                    rest = &rest[e + 1..];
                }
                _ => {
                    out.push(c);
                    rest = &rest[1..];
                }
            }
        } else {
            out.push(c);
            rest = &rest[c.len_utf8()..];
        }
    }
    if code {
        out.push_str("</code>");
    }
    if bold {
        out.push_str("</strong>");
    }
    out
}

fn anchor(title: &str) -> String {
    title
        .chars()
        .filter_map(|c| {
            if c.is_alphanumeric() {
                Some(c.to_ascii_lowercase())
            } else if c == ' ' || c == '-' {
                Some('-')
            } else {
                None
            }
        })
        .collect()
}

/// One HTML page: a table of contents, the sections, figures as `<img>` from `figures/`.
pub fn html(doc: &[Section], title: &str) -> String {
    let mut s = String::new();
    let _ = write!(
        s,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{}</title>\n<style>\n\
         body{{font-family:sans-serif;max-width:1250px;margin:auto;padding:1em;line-height:1.45}}\n\
         table{{border-collapse:collapse;margin:0.6em 0}}td,th{{border:1px solid #bbb;padding:3px 7px;text-align:left;vertical-align:top}}\n\
         th{{background:#eee}}img{{max-width:100%;border:1px solid #ddd}}figure{{margin:1em 0}}\n\
         code{{background:#f4f4f4;padding:0 3px}}.reproduced{{background:#e3f6e3}}.explained{{background:#fff6d6}}.open{{background:#fbe1e1}}\n\
         </style></head><body>\n",
        escape(title)
    );
    s.push_str("<nav><ul>\n");
    for sec in doc.iter().filter(|x| x.level == 2) {
        let _ = writeln!(s, "<li><a href=\"#{}\">{}</a></li>", anchor(&sec.title), escape(&sec.title));
    }
    s.push_str("</ul></nav>\n");
    for sec in doc {
        let l = sec.level.clamp(1, 6);
        let _ = writeln!(s, "<h{l} id=\"{}\">{}</h{l}>", anchor(&sec.title), inline(&sec.title));
        for b in &sec.blocks {
            match b {
                Block::Para(p) => {
                    let _ = writeln!(s, "<p>{}</p>", inline(p));
                }
                Block::Table { header, rows } => {
                    s.push_str("<table><tr>");
                    for h in header {
                        let _ = write!(s, "<th>{}</th>", inline(h));
                    }
                    s.push_str("</tr>\n");
                    for r in rows {
                        s.push_str("<tr>");
                        for c in r {
                            let class = if c.starts_with("reproduced") {
                                " class=\"reproduced\""
                            } else if c.starts_with("differs, explained") {
                                " class=\"explained\""
                            } else if c.starts_with("differs, open") {
                                " class=\"open\""
                            } else {
                                ""
                            };
                            let _ = write!(s, "<td{class}>{}</td>", inline(c));
                        }
                        s.push_str("</tr>\n");
                    }
                    s.push_str("</table>\n");
                }
                Block::Figure { file, caption } => {
                    let _ = writeln!(
                        s,
                        "<figure><img src=\"figures/{}\" alt=\"{}\" loading=\"lazy\"><figcaption>{}</figcaption></figure>",
                        escape(file),
                        escape(caption),
                        inline(caption)
                    );
                }
            }
        }
    }
    s.push_str("</body></html>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inline_markup() {
        assert_eq!(
            inline("a `x<y` **b** [c](d.png)"),
            "a <code>x&lt;y</code> <strong>b</strong> <a href=\"d.png\">c</a>"
        );
        assert_eq!(inline("[not a link"), "[not a link");
    }

    #[test]
    fn markdown_table_escapes_pipes() {
        let doc = [Section {
            level: 2,
            title: "T".into(),
            blocks: vec![Block::Table { header: vec!["a".into()], rows: vec![vec!["x|y".into()]] }],
        }];
        assert_eq!(markdown(&doc), "## T\n\n| a |\n|---|\n| x\\|y |\n\n");
    }
}
